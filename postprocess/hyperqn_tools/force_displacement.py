"""The force-displacement curve of a support from a run's reactions.csv (`output: {reactions: true}`,
docs/outputs.md#reactionscsv): the force the support exerts on the body along an axis, against the
support's travel along it: its moment point p (the centre of its box moved by its motion; the origin
moved so for a support of a face tag alone) minus that point at rest, read from the run's config.yaml.

    /usr/bin/python3 -m hyperqn_tools.force_displacement OUTDIR --support 'fixed[1]' --axis x \\
        --png curve.png --csv curve.csv

Prints the curve's table; --png draws it (a name ending in .png; matplotlib: without it, --png is
refused before anything is printed or written), --csv writes it.
"""
import argparse
import csv
import sys

import os

import numpy as np
import yaml

from hyperqn_tools.cli import ArgumentParser, unwritable_file, writing
from hyperqn_tools.output import read_reactions
from hyperqn_tools.style import NO_MATPLOTLIB, pyplot

AXES = "xyz"


def box_centre(outdir, support):
    """The centre of a support's box at rest, from the run's config.yaml (its box.min and box.max)."""
    path = os.path.join(outdir, "config.yaml")
    try:
        with open(path) as f:
            config = yaml.safe_load(f)
    except OSError as e:
        raise SystemExit(f"{path}: cannot be read ({e.strerror}); the run writes it at its start") from None
    except (yaml.YAMLError, ValueError) as e:
        raise SystemExit(f"{path}: not valid YAML ({' '.join(str(e).split())})") from None
    if not isinstance(config, dict):
        raise SystemExit(f"{path}: not a map of the run's keys")
    lo, hi = config.get(f"{support}.box.min"), config.get(f"{support}.box.max")
    if lo is None and hi is None and config.get(f"{support}.face_tag") is not None:
        return np.zeros(3)  # a support of a face tag alone: its moment point is the origin, moved by its motion
    if lo is None or hi is None:
        raise SystemExit(f"{path} has no {support}.box.min and .max")
    try:
        return (np.array(lo, dtype=float) + np.array(hi, dtype=float)) / 2
    except (TypeError, ValueError):
        raise SystemExit(f"{path}: {support}.box.min and .max are not 3 numbers each") from None


def curve(outdir, support, axis):
    """(travel, force) arrays of one support along axis ('x', 'y' or 'z'), one entry per frame."""
    if not os.path.isfile(os.path.join(outdir, "reactions.csv")):
        raise SystemExit(f"{outdir}/reactions.csv: no such file (the run must have output.reactions: true)")
    try:
        supports = read_reactions(outdir)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    if support not in supports:
        raise SystemExit(f"{outdir}/reactions.csv has no support {support!r}; it has {', '.join(supports)}")
    rows = supports[support]
    k = AXES.index(axis)
    return rows["p" + axis] - box_centre(outdir, support)[k], rows["f" + axis]


def main(argv=None):
    ap = ArgumentParser(prog="python3 -m hyperqn_tools.force_displacement", description=__doc__,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir", help="a run's output directory (with reactions.csv)")
    ap.add_argument("--support", required=True, help="the support's name as reactions.csv gives it, e.g. 'fixed[1]'")
    ap.add_argument("--axis", choices=list(AXES), default="x")
    ap.add_argument("--png", help="draw the curve into this PNG file")
    ap.add_argument("--csv", help="write the curve into this CSV file")
    a = ap.parse_args(argv)
    if a.png and not a.png.lower().endswith(".png"):  # matplotlib would take the name's end for a format
        ap.error(f"--png {a.png}: the figure's name must end in .png")
    for option, path in (("--csv", a.csv), ("--png", a.png)):
        why = path and unwritable_file(path, parents=False)
        if why:  # found before the curve is read and printed
            ap.error(f"{option} {why}")
    if a.png and pyplot() is None:  # the figure asked for cannot be drawn: refused, as an unwritable path
        ap.error(f"--png {a.png}: cannot draw it: {NO_MATPLOTLIB}; leave out --png for the table and --csv")
    travel, force = curve(a.outdir, a.support, a.axis)
    print(f"travel_{a.axis} force_{a.axis}")
    for u, f in zip(travel, force):
        print(f"{u:.9g} {f:.9g}")
    write_curve(a, travel, force, ap)
    return 0


def write_curve(a, travel, force, ap):
    """The curve into a.csv and a.png, those given; a write that fails (a full disk: what
    unwritable_file cannot see) is ap's one-line error naming the file, which is removed."""
    for path, write in ((a.csv, write_csv), (a.png, draw_curve)):
        if not path:
            continue
        try:
            with writing(path):
                write(a, travel, force)
        except OSError as e:
            ap.error(f"cannot write {e.filename}: {e.strerror}")


def write_csv(a, travel, force):
    """The curve into a.csv."""
    with open(a.csv, "w", newline="") as out:
        w = csv.writer(out)
        w.writerow([f"travel_{a.axis}", f"force_{a.axis}"])
        w.writerows(zip(travel, force))


def draw_curve(a, travel, force):
    """The curve drawn into a.png (a PNG whatever matplotlib's default format)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(np.concatenate([[0], travel]), np.concatenate([[0], force]), marker=".")
    ax.set_xlabel(f"travel of {a.support} along {a.axis}")
    ax.set_ylabel(f"force of {a.support} on the body along {a.axis}")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.png, dpi=120, format="png")
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
