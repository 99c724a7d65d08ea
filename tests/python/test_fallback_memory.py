"""The fallback chain's memory of sub-step sizes (solver.keep_substeps, src/model/substep_memory.hpp,
docs/guardrails.md#fallback), end to end on a cube of 6 tets given 1 iteration per attempt, so that
most frames need 2 or 4 sub-steps (the rule itself, frame by frame: tests/test_substep_memory.cpp):
- with the memory, frames start at the size of the frames before ("[k sub-steps, kept]" on the
  console, summary.json's kept_substep_frames) and take fewer iterations; without it (0) none does;
- the memory is part of the run's state: a restart from a checkpoint written while a size is kept
  equals the uninterrupted run bit for bit, at 1 and 2 ranks.
"""
import re

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_checkpoint, read_summary

FRAMES = 30


def cube(frames=FRAMES, **solver):
    return {
        "mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [1, 1, 1]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
        "fixed": [{"box": {"min": [-0.001, -0.001, -0.001], "max": [1.001, 0.001, 1.001]}}],
        "gravity": [0, -9.81, 0],
        "time": {"dt": 0.01, "frames": frames},
        "solver": {"type": "lbfgs", "iterations": 1, "max_iterations": 1, "max_halvings": 2, "newton_fallback": False,
                   **solver},
        "output": {"every": 5},
    }


def run(tmp_path, name, deck, ranks=1, extra=()):
    out = tmp_path / name
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *extra], ranks=ranks)
    return out, proc.stdout


def test_kept_sizes_are_said_and_save_iterations(tmp_path):
    kept, kept_log = run(tmp_path, "kept", cube())
    off, off_log = run(tmp_path, "off", cube(keep_substeps=0))
    s_kept, s_off = read_summary(kept), read_summary(off)
    lines = len(re.findall(r"sub-steps, kept\]", kept_log))
    print(f"kept: {s_kept['iterations']} iterations, {s_kept['substepped_frames']} frames sub-stepped, "
          f"{s_kept['kept_substep_frames']} kept; off: {s_off['iterations']}, {s_off['substepped_frames']}")
    assert s_kept["kept_substep_frames"] == lines > 0
    assert s_off["kept_substep_frames"] == 0 and "kept]" not in off_log and s_off["substepped_frames"] > 0
    assert s_kept["iterations"] < s_off["iterations"]


@pytest.mark.parametrize("ranks", [1, 2])
def test_restart_while_a_size_is_kept_is_bitwise_exact(tmp_path, ranks):
    full, _ = run(tmp_path, "full", cube(), ranks)
    restarted = tmp_path / "restarted"
    run(tmp_path, "first", dict(cube(frames=15), checkpoint={"every": 15}), ranks)
    (tmp_path / "first").rename(restarted)
    saved = read_checkpoint(restarted / "checkpoints" / "checkpoint_15.h5")
    assert saved["substep_halvings"] > 0, saved  # else the restart would test nothing of the memory
    proc = run_hyperqn([write_deck(tmp_path / "then.yaml", cube()), "-o", restarted, "--restart", "latest"], ranks=ranks)
    assert "restart from" in proc.stdout
    a, b = final_frame(full), final_frame(restarted)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.velocity, b.velocity)
    for key in ("iterations", "substepped_frames", "kept_substep_frames"):
        assert read_summary(full)[key] == read_summary(restarted)[key], key

