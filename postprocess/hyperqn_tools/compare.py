#!/usr/bin/env python3
"""Compares the final positions of two hyperqn runs vertex by vertex (e.g. 1 rank vs 2 ranks).

Prints the largest position difference relative to the largest displacement of the first run
(which --rtol, in [0, 1), bounds: exit 1 if it is larger) and relative to the rest shape's
bounding-box diagonal (the measure the docs mostly quote, "of the diagonal"). The two runs must
end at the same frame and time (a run killed early, or of another time step, is not compared:
exit 1 naming both), whatever frames each wrote before it; --any-end compares their last frames
wherever they end (a static answer against a settled dynamic run).

    python3 -m hyperqn_tools.compare RUN_A RUN_B [--rtol 1e-8] [--any-end]
"""
import argparse
import math
import sys

import numpy as np

from hyperqn_tools.cli import ArgumentParser, fraction
from hyperqn_tools.output import last_listed, read_frame, rest_diagonal


def final_frames(dir_a, dir_b, same_end=True):
    """The last frames of two runs of the same mesh, which end at the same frame and time unless not
    same_end (raises ValueError naming both if they do not, or if their vertex sets differ)."""
    (na, ta, pa), (nb, tb, pb) = last_listed(dir_a), last_listed(dir_b)
    if same_end and (na != nb or not math.isclose(ta, tb, rel_tol=1e-9)):
        raise ValueError(f"the runs end at different frames: {dir_a} at frame {na} (t = {ta:.9g}), {dir_b} at "
                         f"frame {nb} (t = {tb:.9g}); a run stopped early, or a run of other time steps?")
    a, b = read_frame(pa, na), read_frame(pb, nb)
    if not np.array_equal(a.vertex_id, b.vertex_id):
        raise ValueError(f"the runs have different vertex sets: {dir_a} ({len(a.vertex_id)} vertices at frame {na}), "
                         f"{dir_b} ({len(b.vertex_id)} at frame {nb}); runs of other meshes?")
    return a, b


def relative_difference(dir_a, dir_b, same_end=True):
    """(max |x_a - x_b| / max |u_a|, max |x_a - x_b|, max |u_a|) over the vertices of the last frames
    (equal positions are 0 apart even where nothing moved; different ones of a body at rest inf);
    same_end as for final_frames."""
    return frame_difference(*final_frames(dir_a, dir_b, same_end))


def frame_difference(a, b):
    """relative_difference of two Frames."""
    diff = np.max(np.linalg.norm(a.points - b.points, axis=1))
    scale = np.max(np.linalg.norm(a.displacement, axis=1))
    if scale == 0:
        return (0.0 if diff == 0 else np.inf), diff, scale
    return diff / scale, diff, scale


def main():
    p = ArgumentParser(prog="python3 -m hyperqn_tools.compare", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run_a")
    p.add_argument("run_b")
    p.add_argument("--rtol", type=fraction, default=1e-8,
                   help="bound of the difference relative to the largest displacement, in [0, 1)")
    p.add_argument("--any-end", action="store_true",
                   help="compare the last frames of runs that end at other frames or times")
    args = p.parse_args()
    try:
        a, b = final_frames(args.run_a, args.run_b, same_end=not args.any_end)
    except (OSError, ValueError) as e:  # no run there, a damaged frame, other meshes: said, not a traceback
        sys.exit(f"compare: {e}")
    rel, diff, scale = frame_difference(a, b)
    diagonal = rest_diagonal(a)
    print(f"max |x_a - x_b| = {diff:.3e}, max |u_a| = {scale:.3e}, relative {rel:.3e} (rtol {args.rtol:g}); "
          f"{diff / diagonal:.3e} of the rest diagonal {diagonal:.3e}")
    sys.exit(0 if rel <= args.rtol else 1)


if __name__ == "__main__":
    main()
