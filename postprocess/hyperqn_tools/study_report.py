#!/usr/bin/env python3
"""Turns `hyperqn study` outputs into the paper's error-against-time figures and tables.

For every study directory given (each holds study.csv, trajectory.csv, study.json; a directory of
a study with `study.integrators` holds one such directory per integrator, and stands for them):
  - error_vs_time.png: relative error e = (g - g*)/(g(x0) - g*) against wall time, both on log
    axes, one panel per study frame, one curve per solver; each curve ends where it reaches
    round-off (see `until_roundoff`), a circle marks the first iterate with e <= 1e-3 and the
    legend gives its time in ms;
  - trajectory.png: RMS vertex error against the converged-Newton trajectory (relative to the
    bounding-box diagonal) against cumulative run time, one curve per solver.
Then one Markdown report (--out, default: report.md beside the first directory's parent) with,
per study and frame, each solver's time to reach e <= 1e-1, 1e-2, 1e-3, 1e-4, 1e-6 and the
speed-up over Newton at each level, plus the trajectory errors and times, and an overview figure
(one panel per study). The figures need matplotlib: without it the report is written with its
tables alone, and one line says the figures were skipped (exit 0).

    PYTHONPATH=postprocess /usr/bin/python3 -m hyperqn_tools.study_report OUTDIR... --out report.md
"""
import argparse
import csv
import json
import math
import os
import sys
from collections import defaultdict

from hyperqn_tools.cli import ArgumentParser, unwritable_file, writing
from hyperqn_tools.style import NO_MATPLOTLIB, pyplot, solver_style

LEVELS = [1e-1, 1e-2, 1e-3, 1e-4, 1e-6]
MARKED_LEVEL = 1e-3  # error_vs_time.png marks where each solver first reaches it
FLOOR = 1e-16  # e below round-off is drawn at this level on the log axis (trajectory.png)
# Where a curve of e stops saying anything: e is computed from g, a sum over many elements with
# cancellation (converged solvers' g jitters by about 40 eps |g| on input/study/bar_neohookean.yaml),
# so e is noise below ROUNDOFF_G eps |g*| / (g(x0) - g*), and never trusted below ROUNDOFF_E.
ROUNDOFF_E = 1e-13
ROUNDOFF_G = 100


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def load_study(directory):
    """{'meta', 'curves': {frame: {solver: [(t, e, grad, it, g)]}}, 'trajectory': {solver: [(frame, t, err)]}}"""
    curves = defaultdict(lambda: defaultdict(list))
    path = os.path.join(directory, "study.csv")
    for line, r in enumerate(read_csv(path), start=2):
        try:
            curves[int(r["frame"])][r["solver"]].append(
                (float(r["time_s"]), float(r["rel_error"]), float(r["grad_norm"]), int(r["iteration"]),
                 float(r["energy"])))
        except (KeyError, TypeError, ValueError) as e:  # a file cut short or edited: said, not a traceback
            sys.exit(f"{path}:{line}: not a row of a study ({type(e).__name__}: {e})")
    trajectory = defaultdict(list)
    stopped = {}  # solver: (frame, why its trajectory stopped)
    tpath = os.path.join(directory, "trajectory.csv")
    if os.path.exists(tpath):
        for line, r in enumerate(read_csv(tpath), start=2):
            try:
                if r.get("status", "ok") != "ok":  # stopped by a guardrail there: no error to plot
                    stopped[r["solver"]] = (int(r["frame"]), r["status"])
                    continue
                trajectory[r["solver"]].append((int(r["frame"]), float(r["time_s"]), float(r["rel_rms_error"])))
            except (KeyError, TypeError, ValueError) as e:  # as study.csv's rows
                sys.exit(f"{tpath}:{line}: not a row of a trajectory ({type(e).__name__}: {e})")
    meta = {}
    if os.path.exists(os.path.join(directory, "study.json")):
        with open(os.path.join(directory, "study.json")) as f:
            try:
                meta = json.load(f)
            except json.JSONDecodeError as e:
                sys.exit(f"{os.path.join(directory, 'study.json')}: not JSON ({e})")
    if not curves:  # empty, or its header alone: a study killed before its first row
        sys.exit(f"{path}: no rows (a study cut short?)")
    meta.setdefault("title", os.path.basename(os.path.normpath(directory)))
    return {"dir": directory, "meta": meta, "curves": curves, "trajectory": trajectory, "stopped": stopped}


def time_to_reach(points, level):
    """Wall time of the first iterate with e <= level, or None."""
    for t, e, *_ in points:
        if e <= level:
            return t
    return None


def roundoff_level(by_solver):
    """The e below which a frame's curves are round-off: max(ROUNDOFF_E, ROUNDOFF_G eps |g*| /
    (g(x0) - g*)), with g(x0) the common start and g* the lowest g any solver reached."""
    energies = [p[4] for pts in by_solver.values() for p in pts]
    g0, g_star = next(iter(by_solver.values()))[0][4], min(energies)
    if not g0 > g_star:
        return ROUNDOFF_E
    return max(ROUNDOFF_E, ROUNDOFF_G * sys.float_info.epsilon * abs(g_star) / (g0 - g_star))


def until_roundoff(points, level):
    """A curve up to its first iterate with e <= level (round-off), or, if it never gets there, up
    to its lowest e: the iterates after that only repeat the same e in noise (or stagnate)."""
    for i, p in enumerate(points):
        if p[1] <= level:
            return points[:i + 1]
    lowest = min(range(len(points)), key=lambda i: points[i][1])
    return points[:lowest + 1]


def ms_label(t):
    ms = 1e3 * t
    return f"{ms:.3g} ms" if ms < 1000 else f"{ms:.0f} ms"


def plot_curves(ax, by_solver, title):
    """log e against log wall time, one curve per solver (not the reference), each up to round-off,
    with its first iterate at e <= MARKED_LEVEL circled and labelled."""
    level = roundoff_level(by_solver)
    bottom = level / 10  # e below round-off is drawn here
    solvers = sorted(s for s in by_solver if s != "reference")
    t_min, t_max = math.inf, 0.0
    for solver in solvers:
        pts = until_roundoff(by_solver[solver], level)
        color, ls = solver_style(solver)
        ts = [1e3 * p[0] for p in pts]
        t_min, t_max = min(t_min, ts[0]), max(t_max, ts[-1])
        reached = next((p for p in pts if p[1] <= MARKED_LEVEL), None)
        # The time goes into the legend: markers of fast solvers lie close together.
        label = f"{solver}: {ms_label(reached[0])}" if reached else f"{solver}: not reached"
        line, = ax.loglog(ts, [max(p[1], bottom) for p in pts], color=color, ls=ls, marker=".", ms=3,
                          label=label)
        if reached:
            ax.plot(1e3 * reached[0], max(reached[1], bottom), "o", ms=8, mfc="none", mec=line.get_color(),
                    mew=1.5)
    for e, text, ls in ((MARKED_LEVEL, f"e = {MARKED_LEVEL:g}", ":"), (level, "round-off", "--")):
        ax.axhline(e, color="0.6", lw=0.6, ls=ls)
        ax.text(0.99, e, text, transform=ax.get_yaxis_transform(), fontsize=7, color="0.4", ha="right",
                va="bottom")
    if t_max > 0:
        ax.set_xlim(t_min / 1.5, t_max * 1.5)
    ax.set_ylim(bottom, 2.0)
    ax.set_xlabel("wall time (ms)")
    ax.set_ylabel("relative error e")
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left", title=f"time to e ≤ {MARKED_LEVEL:g} (○)", title_fontsize=8)


def study_figures(plt, study):
    frames = sorted(study["curves"])
    fig, axes = plt.subplots(1, len(frames), figsize=(5 * len(frames), 4), squeeze=False)
    for ax, frame in zip(axes[0], frames):
        plot_curves(ax, study["curves"][frame], f"{study['meta']['title']}, frame {frame}")
    fig.tight_layout()
    path = os.path.join(study["dir"], "error_vs_time.png")
    with writing(path):
        fig.savefig(path, dpi=120)
    plt.close(fig)
    if study["trajectory"]:
        fig, ax = plt.subplots(figsize=(5, 4))
        for solver, pts in sorted(study["trajectory"].items()):
            color, ls = solver_style(solver)
            ax.semilogy([p[1] for p in pts], [max(p[2], FLOOR) for p in pts], color=color, ls=ls, label=solver)
        ax.set_xlabel("cumulative solve time (s)")
        ax.set_ylabel("RMS vertex error / bbox diagonal")
        ax.set_title(f"{study['meta']['title']}: trajectory vs converged Newton", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = os.path.join(study["dir"], "trajectory.png")
        with writing(path):
            fig.savefig(path, dpi=120)
        plt.close(fig)


def fmt_ms(t):
    return "—" if t is None else f"{1e3 * t:.1f}"


def frame_table(by_solver):
    head = "| solver | " + " | ".join(f"t(e≤{lv:g}) ms" for lv in LEVELS) + " | " + \
        " | ".join(f"speed-up@{lv:g}" for lv in LEVELS) + " |"
    lines = [head, "|" + "---|" * (1 + 2 * len(LEVELS))]
    newton = by_solver.get("newton")
    for solver in sorted(s for s in by_solver if s != "reference"):
        times = [time_to_reach(by_solver[solver], lv) for lv in LEVELS]
        speed = []
        for lv, t in zip(LEVELS, times):
            tn = time_to_reach(newton, lv) if newton else None
            speed.append("—" if t is None or tn is None or t == 0 else f"{tn / t:.1f}×")
        lines.append(f"| {solver} | " + " | ".join(fmt_ms(t) for t in times) + " | " + " | ".join(speed) + " |")
    return lines


def trajectory_table(traj):
    lines = ["| solver | frames | total solve time (s) | final RMS error / diag | max RMS error / diag |", "|---|---|---|---|---|"]
    for solver, pts in sorted(traj.items()):
        lines.append(f"| {solver} | {pts[-1][0]} | {pts[-1][1]:.3f} | {pts[-1][2]:.2e} | {max(p[2] for p in pts):.2e} |")
    return lines


def overview_figure(plt, studies, path):
    n = len(studies)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.5 * cols, 3.8 * rows), squeeze=False)
    for ax, study in zip(axes.flat, studies):
        frame = max(study["curves"])
        plot_curves(ax, study["curves"][frame], f"{study['meta']['title']}, frame {frame}")
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    with writing(path):
        fig.savefig(path, dpi=110)
    plt.close(fig)


def study_directories(paths):
    """The study directories among paths, each directory without a study.csv replaced by its
    sub-directories that have one (a study with an integrator axis), in name order."""
    out = []
    for path in paths:
        if os.path.exists(os.path.join(path, "study.csv")):
            out.append(path)
            continue
        subs = sorted(os.path.join(path, d) for d in os.listdir(path)
                      if os.path.exists(os.path.join(path, d, "study.csv"))) if os.path.isdir(path) else []
        if not subs:
            sys.exit(f"{path}: no study.csv in it nor in a sub-directory")
        out += subs
    return out


def overview_path(out):
    """The report's overview figure, named after it (REPORT_overview.png beside REPORT.md): two
    reports in one directory each keep their own."""
    return os.path.splitext(out)[0] + "_overview.png"


def main():
    p = ArgumentParser(prog="python3 -m hyperqn_tools.study_report", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("studies", nargs="+", help="study output directories")
    p.add_argument("--out", help="Markdown report path (default: <parent of first>/report.md)")
    args = p.parse_args()
    out = args.out or os.path.join(os.path.dirname(os.path.normpath(args.studies[0])), "report.md")
    # Checked before the figures are written: they would be left beside a report never written.
    why = unwritable_file(out) or unwritable_file(overview_path(out))
    if why:
        p.error(f"--out {why}")
    studies = [load_study(d) for d in study_directories(args.studies)]
    lines = ["# Error against time", "",
             "e = (g − g*)/(g(x₀) − g*), g* from Newton converged to ‖∇g‖ ≤ reference_rtol·‖∇g(x₀)‖ "
             "(or the lowest g any solver reached). Times are wall-clock ms from the frame's start; "
             "speed-up = Newton's time / the solver's time to reach the same e. In the figures each curve "
             "ends at its first iterate at round-off (e ≤ max(1e-13, 100 ε|g*|/(g(x₀) − g*)), the dashed "
             "line) or else at its lowest e; circles mark the first iterate with e ≤ 1e-3.", ""]
    try:
        write_report(studies, out, lines)
    except OSError as e:  # what the checks above cannot see (root on a read-only file system)
        p.error(f"cannot write {e.filename}: {e.strerror}")


def write_report(studies, out, lines):
    """The figures of every study (without matplotlib: none, said), the overview and the report at
    out, after lines."""
    plt = pyplot()
    if plt is None:
        lines += [f"Figures skipped: {NO_MATPLOTLIB}.", ""]
    for study in studies:
        if plt:
            study_figures(plt, study)
        m = study["meta"]
        lines += [f"## {m['title']}", ""]
        desc = ", ".join(f"{k} {m[k]}" for k in ("material", "ranks", "vertices", "tets", "dt") if k in m)
        if desc:
            lines += [desc, ""]
        if "stopped" in m:  # a signal ended the study early (docs/study.md, "Signals")
            lines += [f"**Cut short: {m['stopped']}**: the frames and trajectories end there.", ""]
            print(f"study_report: {study['dir']}: the study was cut short ({m['stopped']})", file=sys.stderr)
        elif os.path.exists(os.path.join(study["dir"], "study.json")) and \
                not os.path.exists(os.path.join(study["dir"], "study.h5")):  # hyperqn's: study.h5 written last
            lines += ["**Incomplete: the study did not end** (killed, or still running; no study.h5): "
                      "its frames and trajectories end where it was.", ""]
            print(f"study_report: {study['dir']}: the study did not end (no study.h5: killed, or still running)",
                  file=sys.stderr)
        rel = os.path.relpath(study["dir"], os.path.dirname(out))
        for frame in sorted(study["curves"]):
            lines += [f"### frame {frame}", ""] + frame_table(study["curves"][frame]) + [""]
        lines += [f"![error vs time]({rel}/error_vs_time.png)", ""] if plt else []
        if study["trajectory"]:
            lines += ["### trajectory against converged Newton", ""] + trajectory_table(study["trajectory"]) + \
                     ([""] + ([f"![trajectory]({rel}/trajectory.png)", ""] if plt else []))
        for solver, (frame, why) in sorted(study["stopped"].items()):
            lines += [f"**{solver}: trajectory stopped at frame {frame}** by a guardrail: {why}", ""]
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    overview = overview_path(out)
    if plt:
        overview_figure(plt, studies, overview)
        lines += ["## Overview", "", f"![overview]({os.path.basename(overview)})", ""]
    with writing(out), open(out, "w") as f:
        f.write("\n".join(lines))
    if plt:
        print(f"wrote {out} and {overview}")
    else:
        print(f"wrote {out}")
        print(f"study_report: figures skipped: {NO_MATPLOTLIB}", file=sys.stderr)


if __name__ == "__main__":
    main()
