#!/usr/bin/env python3
"""Compares the final positions of two hyperqn runs vertex by vertex (e.g. 1 rank vs 2 ranks).

Prints the largest position difference relative to the largest displacement of the first run,
and exits non-zero if it exceeds --rtol.
"""
import argparse
import sys

import numpy as np

from hyperqn_output import final_frame


def relative_difference(dir_a, dir_b):
    a, b = final_frame(dir_a), final_frame(dir_b)
    if not np.array_equal(a.vertex_id, b.vertex_id):
        raise ValueError("the runs have different vertex sets")
    diff = np.max(np.linalg.norm(a.points - b.points, axis=1))
    scale = np.max(np.linalg.norm(a.displacement, axis=1))
    return diff / scale, diff, scale


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("run_a")
    p.add_argument("run_b")
    p.add_argument("--rtol", type=float, default=1e-8)
    args = p.parse_args()
    rel, diff, scale = relative_difference(args.run_a, args.run_b)
    print(f"max |x_a - x_b| = {diff:.3e}, max |u_a| = {scale:.3e}, relative {rel:.3e} (rtol {args.rtol:g})")
    sys.exit(0 if rel <= args.rtol else 1)


if __name__ == "__main__":
    main()
