#!/usr/bin/python3
"""The measurements behind the contact defaults (docs/contact.md#defaults): three scenes of a 0.2 m
cube whose answers are known (at rest on level ground: normal force = m g; on a 30 degree incline
with mu = 0.2: acceleration g (sin 30 - mu cos 30); with mu = 0.8: it sticks), each run with the
activation distance at 1e-3 and 1e-2 of the rest diagonal and the warm start at y and at the lower
of y and x_n. Prints a table and writes contact_defaults.csv. Needs postprocess/ on PYTHONPATH.
"""
import argparse, copy, csv, math, os

import numpy as np

from hyperqn_tools import launch
from hyperqn_tools.decks import load_deck, write_deck
from hyperqn_tools.output import read_contact, read_frames, read_summary
from hyperqn_tools.paths import REPO

G = 9.81
DOWN_SLOPE = np.array([-math.sqrt(3) / 2, -0.5, 0.0])


def cube_on_ground():
    return {
        "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [4, 4, 4]}, "transform": {"translate": [-0.1, 0.002, -0.1]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
        "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.5}],
        "gravity": [0, -G, 0], "time": {"dt": 1 / 30, "frames": 45}, "solver": {"type": "lbfgs"},
        "output": {"every": 45},
    }


def incline(name):
    deck = load_deck(os.path.join(REPO, "input", "contact", f"incline_{name}.yaml"))
    deck["output"] = {"every": 5}
    return deck


def slope(out, dt):
    frames = read_frames(out)
    return (np.array([f * dt for f, _ in frames]),
            np.array([frame.displacement.mean(axis=0) @ DOWN_SLOPE for _, frame in frames]))


def measure(scene, out, deck):
    if scene == "rest":
        return f"normal / m g = {read_contact(out)['normal_force'][-1] / (0.2 ** 3 * 1000 * G):.5f}"
    t, s = slope(out, deck["time"]["dt"])
    if scene == "slide":
        late = t >= 0.5
        a = np.linalg.lstsq(np.c_[np.ones(late.sum()), t[late], 0.5 * t[late] ** 2], s[late], rcond=None)[0][2]
        return f"acceleration error {100 * (a / (G * (0.5 - 0.2 * math.sqrt(3) / 2)) - 1):+.2f} %"
    settled = t >= 0.2 - 1e-9
    return f"creep after 0.2 s {1e3 * np.abs(s[settled] - s[settled][0]).max():.3f} mm"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(REPO, "output", "bench-contact-defaults"))
    ap.add_argument("--hyperqn", default=launch.default_binary())
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    scenes = {"rest": cube_on_ground(), "slide": incline("slide"), "stick": incline("stick")}
    rows = []
    for distance in (1e-3, 1e-2):
        for warm in ("inertial", "lower"):
            for scene, base in scenes.items():
                deck = copy.deepcopy(base)
                deck.setdefault("contact", {})
                # a fraction of the rest diagonal D: the bounding box's, after the incline's 30 degree rotation
                diag = {"rest": math.sqrt(3) * 0.2}.get(scene, math.hypot(0.2 * (math.sqrt(3) / 2 + 0.5),
                                                                       0.2 * (math.sqrt(3) / 2 + 0.5), 0.2))
                deck["contact"]["distance"] = distance * diag
                deck["solver"] = {"type": "lbfgs", "warm_start": warm}
                name = f"{scene}-d{distance:g}-{warm}"
                out = os.path.join(args.out, name)
                path = write_deck(os.path.join(args.out, name + ".yaml"), deck)
                launch.run([path, "-o", out], None, args.hyperqn, launch.default_mpiexec(), timeout=1800)
                s = read_summary(out)
                row = {"scene": scene, "distance/D": distance, "warm_start": warm,
                       "friction_velocity": deck["contact"].get("friction_velocity", "default"),
                       "it/frame": round(s["mean_iterations"], 1), "ms/frame": round(s["ms_per_frame"], 2),
                       "extended": s["extended_frames"], "result": measure(scene, out, deck), "status": s["status"]}
                print(row, flush=True)
                rows.append(row)
    with open(os.path.join(args.out, "contact_defaults.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print()
    for r in rows:
        print(" | ".join(str(v) for v in r.values()))


if __name__ == "__main__":
    main()
