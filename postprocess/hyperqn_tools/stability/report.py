"""Stability suite, the report: one row per case and solver (stability.csv), the Markdown report
(stability.md), the verdict grid (verdicts.png) and one figure per case (grad_<case>.png)."""
import csv
import math

import numpy as np

from hyperqn_tools.cli import writing

from hyperqn_tools.stability.judge import (BLOWUP_TOL, MONOTONE_FLOOR, MONOTONE_RTOL, REF_TOL, REST_TOL,
                                           largest_reference_distance, last_frame, reference_ok, rest_distance,
                                           verdict)
from hyperqn_tools.style import NO_MATPLOTLIB, pyplot, solver_style

# What the decks input/stability/initial_*.yaml assume of the top-level `initial:` key (written
# before it existed; src/model/initial_state.cpp now implements it so). A hyperqn that rejects the key
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



COLUMNS = ["case", "solver", "expect", "frames_expected", "frames_completed", "nan", "min_J", "final_min_J",
           "monotone", "g_increase_frames", "roundoff_increase_frames", "ls_failures", "ls_failures_source",
           "ls_roundoff_frames", "converged_frames",
           "max_final_grad_norm", "max_final_grad_rel", "rest_error", "ref_error", "max_ref_error", "mean_iterations", "wall_s",
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
        "max_ref_error": (largest_reference_distance(a, ref)
                          if ref is not None and reference_ok(ref) and expect == "reference" else None),
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
    with writing(path), open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r[k] is None else (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]))
                        for k in COLUMNS})


VERDICT_COLOUR = {"ok": "#4caf50", "degraded": "#ffb300", "failed": "#e53935", "not run": "#9e9e9e"}


def case_figure(case, analyses, verdicts, align, path):
    """Three panels per case: final |grad g| per frame, min J per frame, RMS distance from the rest
    shape per frame; one curve per solver (legend: its verdict) and the reference. Needs matplotlib
    (the suite skips its figures without it)."""
    plt = pyplot()
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(16, 4.2))
    drawn = False
    lowest_J = 0.0
    for solver, a in analyses.items():
        colour, ls = solver_style(solver)
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
    with writing(path):
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
    plt = pyplot()
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
    with writing(path):
        fig.savefig(path, dpi=110)
    plt.close(fig)


def write_markdown(rows, cases, solvers, meta, path):
    """stability.md; meta["figures"] false: written without matplotlib, the figures' links left out."""
    figures = meta.get("figures", True)
    by = {(r["case"], r["solver"]): r for r in rows}
    L = ["# Stability suite", "",
         f"{len(cases)} cases x {len(solvers)} solvers, run by `make stability` "
         f"(`python3 -m hyperqn_tools.stability`) on {meta['ranks']} rank(s), {meta['date']}; total {meta['seconds']:.0f} s.",
         "Each case is a deck in `input/stability/`; every solver runs a copy with only `solver.type` replaced, "
         "so all get the deck's iteration budget (the project defaults: 10 iterations per frame, grad_rtol 1e-6; "
         "Newton too, with its default projected Hessian). Runs: `output/stability/runs/<case>/<solver>/`.",
         "", "![verdicts](verdicts.png)" if figures else f"Figures skipped: {NO_MATPLOTLIB}.", "", "## Verdicts", "",
         "| case | " + " | ".join(solvers) + " |", "|---|" + "---|" * len(solvers)]
    for case in cases:
        cells = []
        for solver in solvers:
            r = by.get((case, solver))
            cells.append(r["verdict"] if r else "–")
        L.append(f"| {case} | " + " | ".join(cells) + " |")
    L += ["", "## Measurements", "",
          "| case | solver | frames | NaN | min J | final min J | monotone | LS fail. | conv. frames | "
          "max final ‖∇g‖ | max final/initial | rest err. | ref. err. | largest ref. err. | it./frame | verdict |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append("| " + " | ".join([
            r["case"], r["solver"], f"{r['frames_completed']}/{r['frames_expected']}", r["nan"], fmt(r["min_J"]),
            fmt(r["final_min_J"]), r["monotone"] or "–",
            fmt(r["ls_failures"]) + (" ᶠ" if r["ls_failures_source"] == "failed_frames" else "")
            + (f" ({r['ls_roundoff_frames']})" if r["ls_roundoff_frames"] else ""),
            fmt(r["converged_frames"]), fmt(r["max_final_grad_norm"]), fmt(r["max_final_grad_rel"]),
            fmt(r["rest_error"]) + (" ◆" if r["expect"] == "rest" else ""),
            fmt(r["ref_error"]) + (" ◆" if r["expect"] == "reference" else ""), fmt(r["max_ref_error"]),
            fmt(r["mean_iterations"]), f"**{r['verdict']}**"]) + " |")
    L += ["", "◆ marks the distance a case is judged by (at the last frame); largest ref. err.: the largest "
          "distance from the converged reference over the frames written. ᶠ: summary.json has no `ls_failures`; "
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
          "is of that size even when g itself is much smaller; a cloth's stiffness times the box's largest face "
          "and strands' axial_stiffness times its diagonal count likewise). Rises below that are counted in the CSV "
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
          "## Figures", ""] + ([] if figures else [f"Skipped: {NO_MATPLOTLIB}."])
    for case in cases if figures else []:
        L.append(f"- [{case}](grad_{case}.png): final ‖∇g‖, min J and distance from rest per frame, every solver"
                 + (" and the reference" if case in refs and refs[case] != "–" else ""))
    with writing(path), open(path, "w") as f:
        f.write("\n".join(L) + "\n")


